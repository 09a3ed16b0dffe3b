"""Interactive 3D views in the browser (viser, ``pip install 'placement[view]'``): a scene with its plan
(robot meshes at each placement, TCP trajectories, base paths, cost maps as floor layers) and a
reachability map as a point cloud. Served on 127.0.0.1 only. Never imported by the algorithms.

``placement.view(target, ...)`` starts one (see :func:`view`); ``placement view`` and ``placement maps
view`` are the commands.
"""

from placement.errors import ViewerError
from placement.viewer.api import view, view_map, view_scene
from placement.viewer.server import View

__all__ = ["View", "ViewerError", "view", "view_map", "view_scene"]
