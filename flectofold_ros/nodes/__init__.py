"""The package's nodes, one per file, each with its ``main`` for ``ros2 run``.

- :mod:`.panel` (``panel_node``) and :mod:`.panel_group` (``panel_group``): panels;
- :mod:`.sun_position` (``sun_position_node``): the sun, and the simulated ``/clock``;
- :mod:`.coordinator` (``coordinator_node``): the schedule;
- :mod:`.rerun_bridge`, :mod:`.bag_recorder`, :mod:`.replay`: observers and playback.

Every ``main`` runs through :func:`flectofold_ros.runtime.runner.run_nodes`.
"""
