"""
A ROS domain of a run's own, on this host only (``inclino demo``).

``choose_private_domain`` listens on candidate domains for other ROS nodes
and returns one on which none is seen (a node of the user's own domain
would otherwise feed the run's node and change its answers);
``isolate_dds`` sets the environment a child node inherits.
"""

import os
import random
import time

#: Domain ids a run may take (0-101 are safe with the default DDS port mapping).
DOMAIN_IDS = range(1, 102)
#: Seconds a domain is listened to for other ROS nodes before it is taken.
LISTEN_S = 1.0


def choose_private_domain(exclude=(), candidates=None, listen_s=LISTEN_S):
    """
    Return a ROS domain id on which no other ROS node is seen, or None.

    Candidates (default: 1..101 from a random start) in ``exclude`` are
    skipped; each is listened to for ``listen_s`` with a node of its own.
    """
    import rclpy
    from rclpy.context import Context
    from rclpy.signals import SignalHandlerOptions

    if candidates is None:
        first = random.randrange(len(DOMAIN_IDS))
        candidates = list(DOMAIN_IDS[first:]) + list(DOMAIN_IDS[:first])
    for domain in candidates:
        if domain in exclude:
            continue
        context = Context()
        rclpy.init(context=context, domain_id=domain,
                   signal_handler_options=SignalHandlerOptions.NO)
        try:
            node = rclpy.create_node('inclino_demo_listener', context=context,
                                     start_parameter_services=False, enable_rosout=False)
            time.sleep(listen_s)   # DDS discovery runs in its own threads
            others = [name for name in node.get_node_names() if name != node.get_name()]
            node.destroy_node()
        finally:
            rclpy.try_shutdown(context=context)
        if not others:
            return domain
    return None


def isolate_dds(log_dir, domain_id=None):
    """
    Keep DDS on this host and on a domain of this run's own; say which.

    ``domain_id`` None: a free one (``choose_private_domain``); RuntimeError
    when none is found.  Logs go under ``log_dir``.
    """
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    os.environ['ROS_LOG_DIR'] = log_dir
    shell = os.environ.get('ROS_DOMAIN_ID')
    if domain_id is not None:
        print(f'== ROS domain {domain_id} (given with --domain-id), this host only')
    else:
        exclude = {int(shell)} if shell and shell.isdigit() else {0}
        domain_id = choose_private_domain(exclude)
        if domain_id is None:
            raise RuntimeError('no free ROS domain found: give one with --domain-id')
        print(f'== ROS domain {domain_id}: a private one (no other ROS node seen on it), this '
              f'host only; ROS_DOMAIN_ID of this shell ({shell or "unset"}) not used '
              '(--domain-id N to choose)')
    os.environ['ROS_DOMAIN_ID'] = str(domain_id)
    return domain_id
