"""A meshcat server that listens on 127.0.0.1 only and exits with its parent.

meshcat 0.3.2's own server binds its web port on every interface and outlives a killed parent.
This launcher binds both ports to 127.0.0.1 and exits when its standard input closes (which
happens when the parent exits, however it exits). Run as ``python -m humanoid._meshcat_server``;
it prints ``zmq_url=...`` and ``web_url=...`` lines. With ``--pages DIR`` it also serves the
files of DIR under ``/humanoid/`` (the live page, same origin as the websocket).
"""

from __future__ import annotations

import os
import sys
import threading


def main() -> None:
    import argparse

    from meshcat.servers.zmqserver import StaticFileHandlerNoCache, ZMQWebSocketBridge

    parser = argparse.ArgumentParser(prog="python -m humanoid._meshcat_server")
    parser.add_argument("--pages", help="a directory served under /humanoid/")
    pages = parser.parse_args().pages

    class LocalBridge(ZMQWebSocketBridge):
        def make_app(self):
            app = super().make_app()
            listen = app.listen

            def local_listen(port, **kwargs):
                kwargs["address"] = "127.0.0.1"
                return listen(port, **kwargs)

            app.listen = local_listen
            if pages:
                page = (r"/humanoid/(.*)", StaticFileHandlerNoCache,
                        {"path": pages, "default_filename": "index.html"})  # fmt: skip
                app.add_handlers(r".*", [page])
            return app

    bridge = LocalBridge(host="127.0.0.1")
    print(f"zmq_url={bridge.zmq_url}", flush=True)
    print(f"web_url={bridge.web_url}", flush=True)

    def watch_parent() -> None:
        sys.stdin.read()  # returns at EOF: the parent closed the pipe or died
        os._exit(0)

    threading.Thread(target=watch_parent, daemon=True).start()
    try:
        bridge.run()
    except KeyboardInterrupt:
        pass


if __name__ == "__main__":
    main()
