"""A site network for the facade's DDS traffic: a site CA, host certificates, Fast DDS profiles.

No rclpy, by rule, as in :mod:`flectofold_ros.wire`: :mod:`.certificates` makes the site's
certificate authority and each host's key and certificate (``cryptography``),
:mod:`.fastdds_profile` writes and checks a host's Fast DDS XML profile (TCPv4 with TLS). The
``site_certificates`` command (:mod:`flectofold_ros.commands.site_certificates`) is their
front end; ``facade --site-profile`` and the launch file's ``site_profile`` take the
profile. Why and how: ``msg_docs/security.md``.
"""
