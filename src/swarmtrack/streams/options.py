"""The live outputs' command-line options (``--foxglove [HOST:PORT]``, ``--ros2``), shared by ``run``, ``live``,
``replay``, ``monitor`` and ``agent``, and the taps they make (:func:`taps_of`)."""

from __future__ import annotations

import errno
import functools
from dataclasses import dataclass

import click

from swarmtrack.cli_support import UsageFailure
from swarmtrack.extras import require

#: Where ``--foxglove`` alone serves (Foxglove's own default port).
FOXGLOVE_DEFAULT = "127.0.0.1:8765"


@dataclass(frozen=True)
class Outputs:
    """The live outputs a command was asked for: ``--foxglove [HOST:PORT]`` (None: none) and ``--ros2`` with its
    namespace and domain."""

    foxglove: str | None = None
    ros2: bool = False
    namespace: str = "uav_{n}"
    domain: int | None = None

    def taps(self, stamp_epoch: float | None = None) -> list:
        """The taps asked for (:func:`taps_of`), said where they are (:func:`announce`)."""
        taps = taps_of(self.foxglove, self.ros2, self.namespace, self.domain, stamp_epoch)
        announce(taps)
        return taps


def output_options(foxglove: bool = True):
    """The options of the live outputs (``--foxglove`` unless ``foxglove`` is False, the ``--ros2`` ones), given to
    the command as one ``outputs`` argument (:class:`Outputs`)."""
    def decorate(f):
        @functools.wraps(f)
        def command(*args, foxglove: str | None = None, ros2: bool = False, ros2_namespace: str = "uav_{n}",
                    ros2_domain: int | None = None, **kwargs):
            return f(*args, outputs=Outputs(foxglove, ros2, ros2_namespace, ros2_domain), **kwargs)

        command = ros2_options(command)
        return foxglove_option(command) if foxglove else command

    return decorate


def foxglove_option(f):
    return click.option("--foxglove", "foxglove", is_flag=False, flag_value=FOXGLOVE_DEFAULT, default=None,
                        metavar="[HOST:PORT]", help=(
                            f"serve the run live to Foxglove (Open connection: ws://HOST:PORT; {FOXGLOVE_DEFAULT} "
                            "when given alone): the scene, the estimates' ellipses, errors and NEES "
                            "(docs/field.md)"))(f)


def ros2_options(f):
    f = click.option("--ros2-domain", type=click.IntRange(0, 232), default=None, metavar="ID",
                     help="--ros2: the DDS domain (default: ROS_DOMAIN_ID, else 0)")(f)
    f = click.option("--ros2-namespace", default="uav_{n}", show_default=True, metavar="NS",
                     help="--ros2: each UAV's namespace, {n} its number (px4_{n} sits beside PX4's topics)")(f)
    return click.option("--ros2", is_flag=True, help=(
        "publish each UAV's estimate (PoseWithCovarianceStamped), pose and setpoint, and the target's truth, as ROS 2 "
        "topics through cyclonedds, no ROS installation needed (docs/field.md)"))(f)


def taps_of(foxglove: str | None = None, ros2: bool = False, namespace: str = "uav_{n}",
            domain: int | None = None, stamp_epoch: float | None = None) -> list:
    """The taps the options ask for (not opened: the recorder opens them); bad input is a
    :class:`~swarmtrack.cli_support.UsageFailure` naming the option."""
    taps: list = []
    ctx = click.get_current_context(silent=True)  # the command that asks: named in a refusal
    who = "" if ctx is None else f"swarmtrack {ctx.info_name} "
    if foxglove is not None:
        require("foxglove", f"{who}--foxglove")
        from swarmtrack.streams.foxglove import FoxgloveView

        host, _, port = foxglove.rpartition(":")
        if not host or not port.isdigit() or not 0 < int(port) < 65536:
            raise UsageFailure(f"--foxglove {foxglove}: expected HOST:PORT, PORT 1..65535 (or --foxglove alone: "
                               f"{FOXGLOVE_DEFAULT})")
        _check_free(host, int(port))
        taps.append(FoxgloveView(host, int(port), stamp_epoch=stamp_epoch))
    if ros2:
        require("ros2", f"{who}--ros2")
        from swarmtrack.streams.ros2 import Ros2Out

        try:
            taps.append(Ros2Out(namespace, domain_id=domain, stamp_epoch=stamp_epoch or 0.0))
        except ValueError as exc:
            raise UsageFailure(f"--ros2-namespace: {exc}") from None
    return taps


def announce(taps: list) -> None:
    """Say where the live outputs are (stderr)."""
    for tap in taps:
        url = getattr(tap, "url", None)
        if url is not None:
            click.echo(f"Foxglove: open connection {url} (Foxglove WebSocket)", err=True)


def _check_free(host: str, port: int) -> None:
    """Refuse ``--foxglove HOST:PORT`` before the run when another program listens there, or HOST is not this
    machine's (the view reports a port taken in between, :class:`~swarmtrack.streams.foxglove.PortInUse`)."""
    import socket

    try:
        with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET, socket.SOCK_STREAM) as s:
            s.bind((host, port))
    except OSError as exc:
        cause = "in use (another program listens there)" if exc.errno == errno.EADDRINUSE else \
            (exc.strerror or str(exc))
        raise UsageFailure(f"--foxglove {host}:{port}: {cause}") from None
