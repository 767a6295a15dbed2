"""ROS 2 shell around :mod:`flectofold_model`: thin nodes, no model logic."""
