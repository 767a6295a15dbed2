"""The facade in Rerun, without rclpy: the scene, its sinks, and bags converted offline.

- :mod:`.scene`: what is logged where (the facade as one batched mesh, sun, series, events)
  from ``/facade/panel_states`` tables;
- :mod:`.sinks`: an ``.rrd`` file, a viewer at an address, or one spawned on 127.0.0.1;
- :mod:`.bag_to_rrd`: a recorded bag through the same scene, with no graph.
"""
