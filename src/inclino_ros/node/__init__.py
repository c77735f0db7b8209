"""The ROS 2 node: adapts messages, parameters, services and QoS to the pipeline; no math here."""
