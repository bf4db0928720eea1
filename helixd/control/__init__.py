"""Pure control core: no sockets, clocks or logging in here.

Imports only the base layer (:mod:`helixd.base`) and numpy; its tunables arrive through the
read-only Protocols of :mod:`helixd.control.params`, which the config models satisfy.
"""
