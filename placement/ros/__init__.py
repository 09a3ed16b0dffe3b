"""ROS 2 face of the planner: ``placement ros serve`` and MCAP recordings of plans.

Needs the ``ros`` extra (``pip install 'placement[ros]'``: rclpy, Fast DDS and the standard message
packages as PyPI wheels, no ROS install). :mod:`placement.ros.live` (the live planner behind the
node) needs none of it; the other modules import the message packages, so import them only after
:func:`require_ros`.
"""

from __future__ import annotations

from placement.errors import PlacementError

#: What to install for the ROS 2 commands.
INSTALL_HINT = "pip install 'placement[ros]'"


def require_ros(what: str) -> None:
    """PlacementError naming ``what`` and how to install the extra, unless rclpy and the messages import."""
    try:
        import geometry_msgs.msg  # noqa: F401
        import nav_msgs.msg  # noqa: F401
        import rclpy  # noqa: F401
        import visualization_msgs.msg  # noqa: F401
    except ImportError as exc:
        raise PlacementError(f"{what} needs ROS 2's Python packages ({exc.name} is missing): {INSTALL_HINT}") from None
