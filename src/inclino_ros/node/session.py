"""
An rclpy session of a live command of its own, spun by hand (``inclino`` live commands, demo).

A LiveSession is one rclpy node; rclpy is initialised without its signal
handlers (as the node is): Ctrl-C raises KeyboardInterrupt in Python, and
SIGTERM (``kill``, what a script sends to a background job) is turned into
the same, so each command ends cleanly and says what it did, never with a
traceback; its teardown never hangs (``live_command``, ``_exit_later``).  A
DemoSession (``inclino demo``) replays bag segments to the node and records
its surveys.  rclpy is imported only when a session starts.
"""

import ctypes
import functools
import os
import signal
import sys
import time

from inclino_ros.io.bag import IMU
from inclino_ros.io.timing import Timeline
from inclino_ros.node.playback import publish_timed
import numpy as np

#: Seconds the rclpy teardown of a live command may take before a watchdog ends the process
#: with the command's exit code: milliseconds normally, 24 minutes once under ~90 concurrent
#: calls (issue 21).
TEARDOWN_S = 20

#: Seconds a read-only or idempotent request waits for its answer before it is first sent
#: again (doubled after each resend; ``LiveSession.answer``).
RESEND_S = 1.0
#: Seconds between two checks that the node is still there while a request waits.
ALIVE_CHECK_S = 1.0


def node_name(name):
    """Return a node name as a full name: ``inclinometer`` -> ``/inclinometer``."""
    return '/' + name.strip('/')


def domain_hint():
    """Return what to check when the node cannot be found, naming this shell's settings."""
    domain = os.environ.get('ROS_DOMAIN_ID', '0 (unset)')
    scope = os.environ.get('ROS_AUTOMATIC_DISCOVERY_RANGE', 'SUBNET (unset)')
    return (f'is inclinometer_node running, and started with the same ROS_DOMAIN_ID '
            f'(this shell: {domain}) and ROS_AUTOMATIC_DISCOVERY_RANGE (this shell: {scope})?')


class LiveSession:
    """One rclpy node of a live command; use as a context manager."""

    def __init__(self, name):
        """
        Initialise rclpy (no signal handlers) and create node ``name``.

        What the DDS layer prints goes to stderr (``_DdsOutputToStderr``): with
        dozens of commands starting at once, Fast DDS's shared-memory port locks
        collide and it prints "RTPS_TRANSPORT_SHM Error ... open_and_lock_file
        failed" on stdout, before the answer a script reads.
        """
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.signals import SignalHandlerOptions

        self._stdout = _DdsOutputToStderr()
        self._previous_term = signal.signal(signal.SIGTERM, _interrupt)
        rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
        self.node = rclpy.create_node(name, start_parameter_services=False)
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)

    def __enter__(self):
        """Return the session."""
        return self

    def __exit__(self, *exc_info):
        """Close the session now, or when the running ``live_command`` returns its exit code."""
        if _CLOSING:
            _CLOSING[-1].append(self)
        else:
            self.close(1)

    def close(self, code):
        """
        Destroy the node, shut rclpy down, restore SIGTERM; never hang there.

        What the command says is said by now (flushed).  The teardown runs in
        the DDS layer, where Python's signal handlers never run: under ~90
        concurrent calls one caller spun in ``destroy_node`` for 24 minutes,
        deaf to SIGTERM (1 of 40 for 20 s, its answer printed).  So during it
        SIGTERM and SIGINT kill the process (their default action, taken by
        the kernel), and after ``TEARDOWN_S`` a watchdog outside Python ends
        the process with the command's exit ``code`` (``_exit_later``),
        whatever the DDS layer does.  In order: the executor first (nothing
        spins any more), then the node, then the context.
        """
        import rclpy
        for stream in (sys.stdout, sys.stderr):
            stream.flush()
        previous_int = signal.signal(signal.SIGINT, signal.SIG_DFL)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        cancel = _exit_later(TEARDOWN_S, code)
        try:
            self.executor.shutdown()
            self.node.destroy_node()
            rclpy.try_shutdown()
        finally:
            cancel()
            signal.signal(signal.SIGINT, previous_int)
            signal.signal(signal.SIGTERM, self._previous_term)
            self._stdout.restore()

    def spin(self, seconds):
        """Process callbacks for ``seconds``."""
        end = time.monotonic() + seconds
        while (left := end - time.monotonic()) > 0:
            self.executor.spin_once(timeout_sec=min(left, 0.05))

    def spin_until(self, done, timeout_s, step_s=0.05):
        """Spin until ``done()`` or ``timeout_s`` passed (None: no limit); return ``done()``."""
        end = None if timeout_s is None else time.monotonic() + timeout_s
        while not done():
            if end is not None and time.monotonic() >= end:
                break
            self.executor.spin_once(timeout_sec=step_s)
        return done()

    def wait_heard_by(self, target, timeout_s, ready_s=None):
        """
        Wait until node ``target`` has discovered this session's endpoints; return whether it did.

        A request (and an answer) goes only to the endpoints the other side
        has discovered: rmw_fastrtps drops a service's answer when it has not
        matched the client's response reader within 100 ms ("failed to send
        response (timeout)"), and a request sent before the node matched the
        client's request writer never reaches it.  Under load the node's
        discovery lags the client's own (``service_is_ready`` sees only that):
        3 of 40 concurrent calls lost their answer, 6 of 40 their request.  A
        node learns a participant's writers, and its readers, in the order
        they were made: so an answer of the node's read-only
        ``~/list_parameters`` to a client made after the caller's own proves
        the node has matched both endpoints of every client made before.
        That request is resent until answered, within ``timeout_s`` (the
        node's name in the graph comes later still: not waited for).  A node
        whose ``~/list_parameters`` is not seen within ``ready_s`` (None:
        ``timeout_s``) has none (the ros2 CLI's): False at once.
        """
        from rcl_interfaces.srv import ListParameters

        end = time.monotonic() + timeout_s
        client = self.node.create_client(ListParameters, f'{node_name(target)}/list_parameters')
        try:
            if not self.spin_until(client.service_is_ready,
                                   timeout_s if ready_s is None else min(ready_s, timeout_s)):
                return False
            answered, _ = self.answer(
                lambda: client.call_async(ListParameters.Request(
                    prefixes=['inclino_ping'], depth=1)), lambda: end, resend=True)
            return answered is not None
        finally:
            self.node.destroy_client(client)

    def answer(self, send, deadline, resend, check=lambda: None):
        """
        Send a request with ``send()`` (it returns the future) and spin until it is answered.

        Return (the answered future, or None once the monotonic time
        ``deadline()`` passed first; the number of requests sent).
        ``resend``: the request is read-only or idempotent, so it is sent
        again after RESEND_S, 2 RESEND_S, 4 RESEND_S, ... without an answer
        (a lost request or answer costs a resend, not the call); no other
        request is ever sent twice.  ``check()`` runs about every
        ALIVE_CHECK_S while waiting (it raises to give up).
        """
        futures = [send()]

        def answered():
            return next((future for future in futures if future.done()), None)

        resend_after_s, sent = RESEND_S, time.monotonic()
        while answered() is None:
            now, end = time.monotonic(), deadline()
            if now >= end:
                return None, len(futures)
            step = min(end - now, ALIVE_CHECK_S)
            if resend:
                step = min(step, max(0.0, sent + resend_after_s - now))
            if self.spin_until(lambda: answered() is not None, step):
                break
            check()
            if resend and time.monotonic() >= sent + resend_after_s:
                futures.append(send())
                sent, resend_after_s = time.monotonic(), 2.0 * resend_after_s
        return answered(), len(futures)

    def other_nodes(self):
        """Return the full names of the ROS nodes this session sees, itself left out."""
        own = self.node.get_fully_qualified_name()
        return sorted(f'{ns.rstrip("/")}/{name}'
                      for name, ns in self.node.get_node_names_and_namespaces()
                      if f'{ns.rstrip("/")}/{name}' != own)

    def not_found(self, what):
        """Return the message for a node that did not answer: what, where, what to check."""
        seen = self.other_nodes()
        return (f'{what}; {domain_hint()} Nodes seen: '
                + (', '.join(seen) if seen else 'none'))


def _interrupt(signum, frame):
    raise KeyboardInterrupt


class _DdsOutputToStderr:
    """
    While it lasts, file descriptor 1 is stderr's; Python's ``sys.stdout`` keeps the real stdout.

    The DDS layer (C++) writes its log to descriptor 1; the command's own
    output goes through ``sys.stdout``, now a copy of the original descriptor.
    """

    def __init__(self):
        """Swap: descriptor 1 to stderr, ``sys.stdout`` to a duplicate of the original."""
        self.stream = sys.stdout
        self.saved = None
        try:
            fileno = self.stream.fileno()
        except (AttributeError, OSError, ValueError):   # no file (a test's buffer)
            return
        self.stream.flush()
        self.saved = os.dup(fileno)
        sys.stdout = open(os.dup(self.saved), 'w', encoding=self.stream.encoding,
                          errors=self.stream.errors,
                          buffering=1 if self.stream.line_buffering else -1)
        os.dup2(sys.stderr.fileno(), fileno)

    def restore(self):
        """Put descriptor 1 and ``sys.stdout`` back."""
        if self.saved is None:
            return
        sys.stdout.flush()
        sys.stdout.close()
        os.dup2(self.saved, self.stream.fileno())
        os.close(self.saved)
        self.saved = None
        sys.stdout = self.stream


#: Per running ``live_command``: the sessions to close once it has its exit code.
_CLOSING = []


def live_command(run):
    """Decorate a live command's ``run(args)``: its sessions close after it, with its exit code."""
    @functools.wraps(run)
    def wrapped(args):
        _CLOSING.append([])
        code = 1   # what main() answers for an exception
        try:
            code = run(args)
            return code
        finally:
            for session in _CLOSING.pop():
                session.close(code)
    return wrapped


class _SigEvent(ctypes.Structure):
    """``struct sigevent`` of Linux (64 bytes) for SIGEV_THREAD."""

    _fields_ = [('value', ctypes.c_void_p), ('signo', ctypes.c_int), ('notify', ctypes.c_int),
                ('function', ctypes.c_void_p), ('attribute', ctypes.c_void_p),
                ('_pad', ctypes.c_int * 8)]


class _TimerSpec(ctypes.Structure):
    """``struct itimerspec``: no interval, a first expiry in whole seconds."""

    _fields_ = [('interval_s', ctypes.c_long), ('interval_ns', ctypes.c_long),
                ('value_s', ctypes.c_long), ('value_ns', ctypes.c_long)]


_SIGEV_THREAD = 2
_CLOCK_MONOTONIC = 1


def _exit_later(seconds, code):
    """
    End the process with exit ``code`` after ``seconds`` unless cancelled; return the canceller.

    A POSIX timer that calls ``_exit(code)`` in a thread of the C library's
    own (SIGEV_THREAD): it needs neither Python's lock nor its signal
    handlers, both unreachable while the DDS layer spins.  Where there is no
    such timer, the kernel's ``alarm`` ends the process instead (exit status
    128 + SIGALRM).
    """
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        event = _SigEvent(value=int(code), notify=_SIGEV_THREAD,
                          function=ctypes.cast(libc._exit, ctypes.c_void_p).value)
        timer = ctypes.c_void_p()
        if libc.timer_create(_CLOCK_MONOTONIC, ctypes.byref(event), ctypes.byref(timer)) != 0:
            raise OSError(ctypes.get_errno(), 'timer_create failed')
        if libc.timer_settime(timer, 0, ctypes.byref(_TimerSpec(value_s=int(seconds))),
                              None) != 0:
            libc.timer_delete(timer)
            raise OSError(ctypes.get_errno(), 'timer_settime failed')
    except (AttributeError, OSError):   # no POSIX timers here
        previous = signal.signal(signal.SIGALRM, signal.SIG_DFL)
        signal.alarm(int(seconds))

        def cancel_alarm():
            signal.alarm(0)
            signal.signal(signal.SIGALRM, previous)
        return cancel_alarm
    return lambda: libc.timer_delete(timer)


class DemoSession(LiveSession):
    """The demo's own rclpy node: replays bag segments, records the node's surveys."""

    def __init__(self, rate):
        """Create the publisher, the survey recorder and the service client; replay at ``rate``."""
        from geometry_msgs.msg import Vector3Stamped
        from rclpy.qos import QoSProfile
        from sensor_msgs.msg import Imu
        from std_srvs.srv import Trigger

        super().__init__('inclino_demo')
        self.rate = rate
        self.publisher = self.node.create_publisher(Imu, 'imu/data_raw', QoSProfile(depth=1000))
        self.surveys = {}
        self.survey_sub = self.node.create_subscription(
            Vector3Stamped, 'survey', self._on_survey, QoSProfile(depth=1000))
        self.client = self.node.create_client(Trigger, '/inclinometer/calibrate_level')
        self.trigger = Trigger.Request

    def _on_survey(self, msg):
        stamp_ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        self.surveys[stamp_ns] = (msg.vector.x, msg.vector.y, msg.vector.z)

    def wait_for_node(self, timeout_s=30.0):
        """Wait until the node's subscription, survey and service are matched."""
        if not self.spin_until(lambda: (self.publisher.get_subscription_count()
                                        and self.client.service_is_ready()
                                        and self.survey_sub.get_publisher_count()),
                               timeout_s):
            raise RuntimeError('inclinometer_node did not come up')
        self.spin(0.3)

    def play(self, series):
        """Publish an ImuSeries with its timing (``rate`` times faster)."""
        publish_timed(Timeline.of([('imu/data_raw', IMU, series)]),
                      {'imu/data_raw': self.publisher}, self.rate,
                      lambda seconds: self.spin(min(seconds, 0.01)))

    def replay(self, series):
        """Publish an ImuSeries with its timing; return the node's surveys of it (N, 3)."""
        self.surveys = {}
        self.play(series)
        self.spin(0.5)
        answers = np.array([self.surveys.get(stamp, (np.nan,) * 3)
                            for stamp in series.stamps_ns.tolist()])
        print(f'   {np.count_nonzero(np.isfinite(answers[:, 0]))} of {series.stamps_ns.size} '
              'surveys received')
        return answers

    def calibrate_during(self, series):
        """Call ~/calibrate_level while the level segment plays; return the answer."""
        future = self.client.call_async(self.trigger())
        self.play(series)
        self.spin_until(future.done, 15.0)
        return future.result() if future.done() else None
