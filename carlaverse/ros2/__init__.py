"""ROS 2 over Zenoh: the session as ROS 2 topics in rmw_zenoh's key and CDR format, and a ROS 2
stack (an automated vehicle) as a participant."""
