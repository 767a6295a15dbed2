"""Command-line front ends that start without rclpy: ``fold_table``, ``day_report``, ``replay``.

``replay`` imports rclpy (:mod:`flectofold_ros.nodes.replay`) only to play a bag onto the
graph; ``replay --to-rrd`` converts offline without it.
"""
