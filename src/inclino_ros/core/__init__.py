"""Pure math of the three seeds: numpy over N samples, no I/O, no ROS."""
