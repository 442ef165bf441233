"""The names the design page answers to: a request for any other ``Host`` is refused.

A page on 127.0.0.1 is still reachable from a web site by DNS rebinding: the site's name is
made to resolve to 127.0.0.1, and the browser then sends the site's requests here with the
site's name in ``Host``. Bokeh checks the ``Origin`` of the websocket only; the page itself,
with its session token, would be served to any name. So every HTTP request (the websocket's
first one too) is answered only for the served address and this machine's own names, checked
before any of Bokeh's or Panel's handlers (:func:`refuse_other_hosts`).
"""
from __future__ import annotations

import socket

from tornado.httputil import HTTPServerRequest
from tornado.routing import Matcher, Rule
from tornado.web import Application, RequestHandler

#: Names of this machine that a page served on it always answers to (a DNS rebinding cannot
#: send them: the browser sends the name it was given, the attacker's).
LOOPBACK_NAMES = ("localhost", "127.0.0.1")
#: Addresses that serve on every interface: the page then also answers to this machine's host
#: name and fully qualified name.
EVERY_INTERFACE = ("", "0.0.0.0", "::")
#: HTTP status of a request for a name the page does not answer to (Forbidden).
REFUSED_STATUS = 403


def _netloc(name: str, port: int) -> str:
    """``name:port`` as a ``Host`` header writes it (an IPv6 address in brackets)."""
    return f"[{name}]:{port}" if ":" in name else f"{name}:{port}"


def served_hosts(address: str, port: int) -> frozenset[str]:
    """The ``Host`` values (lower case, with the port; without it on port 80, which browsers
    leave out) of a page served on ``address``:``port``: the loopback names, the address (the
    browser opened on ``0.0.0.0`` sends that), and for an address on every interface
    (:data:`EVERY_INTERFACE`) this machine's names."""
    names = {*LOOPBACK_NAMES, address.lower()} - {""}
    if address in EVERY_INTERFACE:
        names |= {socket.gethostname().lower(), socket.getfqdn().lower()}
    hosts = {_netloc(name, port) for name in names}
    if port == 80:
        hosts |= {_netloc(name, port).rpartition(":")[0] for name in names}
    return frozenset(hosts)


class _OtherHost(Matcher):
    """Matches a request whose ``Host`` is none of ``hosts``."""

    def __init__(self, hosts: frozenset[str]):
        self.hosts = hosts

    def match(self, request: HTTPServerRequest) -> dict | None:
        return None if request.host.lower() in self.hosts else {}


class _Refused(RequestHandler):
    """Answers every method with :data:`REFUSED_STATUS` and a line saying why."""

    def prepare(self) -> None:
        self.set_status(REFUSED_STATUS)
        self.set_header("Content-Type", "text/plain; charset=utf-8")
        self.finish("cadcam design page: this server answers only to the address it serves on "
                    "(http://127.0.0.1:PORT/ by default)\n")


def refuse_other_hosts(app: Application, hosts: frozenset[str]) -> None:
    """Make ``app`` answer a request whose ``Host`` is none of ``hosts`` with
    :data:`REFUSED_STATUS`, before any handler of its own (its first routing rule)."""
    rules = app.default_router.rules
    app.default_router.add_rules([Rule(_OtherHost(hosts), _Refused)])
    rules.insert(0, rules.pop())


__all__ = ["REFUSED_STATUS", "refuse_other_hosts", "served_hosts"]
