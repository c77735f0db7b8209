"""
The node's sample path: samples taken serialized, in batches, in a thread of their own.

A relay pays rclpy's executor (a new wait set over every entity of the node,
~150 us) and a message conversion for every sample.  Here the input
subscriptions are not waited on by the executor (``ServedElsewhere``): a
``BatchWaker`` thread waits on them alone (a bare rcl wait set, the GIL
released) and, as soon as a sample waits (or ``period_s`` after it, if
asked), runs the node's batch callback itself, holding the node's
``callback_lock``: the callback takes every queued message serialized
(``take_serialized``), decodes the batch at once (``io.bag.decode``) and
publishes bytes encoded the same way.  No executor wake-up per batch; the
executor runs every other callback of the node under the same lock
(``node.executor.spin``), so node state is never touched by two threads at
once.  Batches grow by themselves: what arrives while one is corrected waits
in the queue and is the next batch.  A failure of the callback is raised in
the executor's thread, as a callback's would be (the node stops).
"""

from contextlib import ExitStack
import threading

from inclino_ros.io.bag import BagError, concatenate, decode
from rclpy.callback_groups import CallbackGroup
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.serialization import deserialize_message, serialize_message

#: Longest wait of the waker before it checks whether it should stop [ns].
WAIT_SLICE_NS = 100_000_000


class ServedElsewhere(CallbackGroup):
    """A callback group the executor never runs: its entities are served by a BatchWaker."""

    def can_execute(self, entity):
        """Return False: the executor leaves these entities out of its wait set."""
        return False

    def beginning_execution(self, entity):
        """Return False: never executed by an executor."""
        return False

    def ending_execution(self, entity):
        """Nothing to release."""


class BatchWaker:
    """Runs ``callback`` once per batch of samples on ``subscriptions``, in its own thread."""

    def __init__(self, node, subscriptions, period_s, callback, lock):
        """
        Call ``callback()`` under ``lock`` once samples wait (``period_s`` after the first).

        ``subscriptions`` must be in a ``ServedElsewhere`` group; ``lock`` is
        the one the executor holds while it runs the node's other callbacks.
        """
        self._subscriptions = subscriptions
        self._period_s = period_s
        self._callback = callback
        self._lock = lock
        self._failure = None
        self._stop = threading.Event()
        self._context = node.context
        self._guard = node.create_guard_condition(self._raise_failure)
        self._thread = threading.Thread(target=self._wait_loop, name='inclino-samples',
                                        daemon=True)
        self._thread.start()

    def _raise_failure(self):
        """Raise, in the executor's thread, what the batch callback raised."""
        raise self._failure

    def _wait_loop(self):
        # rclpy (7.1, Jazzy) has no public wait set.  Its public ways to wait cost what this
        # thread is for avoiding, or cannot batch: an Executor builds a new wait set over
        # every entity of its nodes at each spin_once (~0.15 ms) and runs one callback per
        # message, deserialized; rclpy.wait_for_message creates and destroys a subscription
        # per call (messages between calls are lost) and takes one message; the
        # experimental EventsExecutor also runs one callback per message.  What is used
        # here is the binding rclpy's own public wait_for_message and executors are
        # built on (rclpy/wait_for_message.py, executors.py), with the handles held as
        # they hold them; ros-constraints.txt pins the rclpy it was written against.
        wait_set = _rclpy.WaitSet(len(self._subscriptions), 0, 0, 0, 0, 0,
                                  self._context.handle)
        while not self._stop.is_set():
            with ExitStack() as in_use:   # no handle destroyed while waited on
                in_use.enter_context(self._context.handle)
                wait_set.clear_entities()
                for subscription in self._subscriptions:
                    in_use.enter_context(subscription.handle)
                    wait_set.add_subscription(subscription.handle)
                wait_set.wait(WAIT_SLICE_NS)
            if not wait_set.get_ready_entities('subscription'):
                continue
            if self._period_s > 0.0 and self._stop.wait(self._period_s):
                break
            try:
                with self._lock:
                    if self._stop.is_set():
                        break
                    self._callback()
            except Exception as err:  # raised again in the executor's thread
                self._failure = err
                self._guard.trigger()
                break

    def stop(self):
        """End the thread (before the subscriptions are destroyed)."""
        self._stop.set()
        self._thread.join()


def take_serialized(subscription, limit):
    """Return up to ``limit`` CDR messages queued on ``subscription`` (bytes), without waiting."""
    messages = []
    with subscription.handle:
        while len(messages) < limit:
            taken = subscription.handle.take_message(subscription.msg_type, True)
            if taken is None:
                break
            messages.append(taken[0])
    return messages


def _decode_one_way_or_other(messages, msgtype, ros_type):
    """Return the series of ``messages``: as little-endian CDR, else through rclpy."""
    try:
        return decode(messages, msgtype)
    except BagError:
        return decode([serialize_message(deserialize_message(m, ros_type)) for m in messages],
                      msgtype)


def decode_messages(messages, msgtype, ros_type, dropped=None):
    """
    Return the series (``io.bag``) of CDR ``messages`` of ``ros_type`` (``msgtype`` its name).

    The batch decoder reads little-endian CDR; messages of another encoding
    (a big-endian sender) go through rclpy's deserializer first.  A message
    neither reads (a stamp with nanosec >= 1e9: no time) is left out, its
    reason appended to ``dropped`` (a list), so one bad sender's message never
    takes the batch, or the node, with it.
    """
    try:
        return _decode_one_way_or_other(messages, msgtype, ros_type)
    except BagError:
        pass
    kept = []
    for message in messages:
        try:
            kept.append(_decode_one_way_or_other([message], msgtype, ros_type))
        except BagError as err:
            if dropped is not None:
                dropped.append(str(err))
    return concatenate(kept) if kept else decode([], msgtype)
