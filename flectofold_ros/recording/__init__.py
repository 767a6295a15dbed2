"""Bags on disk, without rclpy: crash-tolerant rosbag2 (MCAP) writing, and reading them back.

- :mod:`.bag_segments`: the rotated, crash-tolerant writer and the readers (topics, messages,
  CDR decoding).
"""
