"""A meshcat window with no server: it records the scene and renders meshcat's static HTML.

``meshcat.Visualizer(window=StaticWindow())`` draws into a scene tree kept exactly as meshcat's ZMQ
server keeps it (``meshcat/servers/zmqserver.py``: ``handle_zmq`` updates a
``meshcat.servers.tree.SceneTree``; ``get_scene`` replays it into one HTML page with the viewer's
JavaScript inlined). So ``visualizer.static_html()`` gives the same self-contained page the server
would, without starting a process, opening a port or touching the network.

meshcat is imported here at module level: import this module only where meshcat is wanted.
"""

from __future__ import annotations

import os

import umsgpack
from meshcat.servers.tree import SceneTree, find_node, walk
from meshcat.servers.zmqserver import MESHCAT_COMMANDS, VIEWER_ROOT, create_command

# The page meshcat's server renders for "get_scene" (zmqserver.py), verbatim.
_PAGE = """
                <!DOCTYPE html>
                <html>
                    <head> <meta charset=utf-8> <title>MeshCat</title> </head>
                    <body>
                        <div id="meshcat-pane">
                        </div>
                        <script>
                            {mainminjs}
                        </script>
                        <script>
                            var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
                            {commands}
                        </script>
                         <style>
                            body {{margin: 0; }}
                            #meshcat-pane {{
                                width: 100vw;
                                height: 100vh;
                                overflow: hidden;
                            }}
                        </style>
                        <script id="embedded-json"></script>
                    </body>
                </html>
            """


def _viewer_javascript() -> str:
    with open(os.path.join(VIEWER_ROOT, "main.min.js")) as handle:
        return handle.read()


class StaticWindow:
    """A stand-in for ``meshcat.visualizer.ViewerWindow`` that records instead of sending.

    Attributes:
        tree: the scene tree (``meshcat.servers.tree.SceneTree``), updated as the server does.
        web_url: always None (there is no server).
    """

    web_url = None

    def __init__(self) -> None:
        self.tree = SceneTree()

    def send(self, command) -> None:
        """Apply one meshcat command (anything with ``lower()``) to the scene tree."""
        data = command.lower()
        self.apply(data["type"], data["path"], umsgpack.packb(data))

    def apply(self, cmd: str, path_text: str, payload: bytes) -> None:
        """The scene-tree update of ``ZMQWebSocketBridge.handle_zmq`` for one command."""
        if cmd not in MESHCAT_COMMANDS:
            raise ValueError(f"unsupported meshcat command {cmd!r} for a static scene")
        path = [p for p in path_text.split("/") if p]
        if cmd == "set_transform":
            find_node(self.tree, path).transform = payload
        elif cmd == "set_object":
            node = find_node(self.tree, path)
            node.object = payload
            node.properties = []
        elif cmd == "set_property":
            find_node(self.tree, path).properties.append(payload)
        elif cmd == "set_animation":
            find_node(self.tree, path).animation = payload
        elif cmd == "delete":
            if path:
                parent = find_node(self.tree, path[:-1])
                if path[-1] in parent:
                    del parent[path[-1]]
            else:
                self.tree = SceneTree()

    def get_scene(self) -> str:
        """The self-contained HTML page of the scene (what the server's ``get_scene`` returns)."""
        commands = []
        for node in walk(self.tree):
            if node.object is not None:
                commands.append(create_command(node.object))
            for prop in node.properties:
                commands.append(create_command(prop))
            if node.transform is not None:
                commands.append(create_command(node.transform))
            if node.animation is not None:
                commands.append(create_command(node.animation))
        return _PAGE.format(mainminjs=_viewer_javascript(), commands="".join(commands))

    def node(self, path: str):
        """The tree node at ``path`` (e.g. ``"/meshcat/pincal/ghosts"``), or KeyError."""
        node = self.tree
        for part in (p for p in path.split("/") if p):
            if part not in node:
                raise KeyError(path)
            node = node[part]
        return node

    # The rest of ViewerWindow's interface, for a window without a browser.
    def open(self) -> StaticWindow:
        raise RuntimeError("a static meshcat scene has no server to open: save its static_html()")

    def wait(self) -> str:
        raise RuntimeError("a static meshcat scene has no server: no browser can connect")

    def get_image(self, *args, **kwargs):
        raise RuntimeError("a static meshcat scene cannot capture images: open its HTML in a browser")

    def close(self) -> None:
        """Nothing to close."""

    def __repr__(self) -> str:
        return f"StaticWindow({sum(1 for _ in walk(self.tree))} nodes)"
