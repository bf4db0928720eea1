"""Pure control core: no sockets, clocks or logging in here."""
