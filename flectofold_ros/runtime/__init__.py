"""How the package's processes run on ROS: executables, runner, interfaces, parameters.

The executables' one list and their entry points (:mod:`.executables`), the process runner
with its signal handling (:mod:`.runner`, rclpy imported when a node is run), the message
types of the contract (:mod:`.interfaces`), the nodes' parameter specs (:mod:`.parameters`),
the ``/diagnostics`` statuses (:mod:`.diagnostics`) and the watch for another facade on the
domain (:mod:`.domain_watch`).
"""
