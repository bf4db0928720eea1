"""helixd.link.services: the autopilot's services over the link, each an exchange of requests
and answers (commands and actions, parameters, the mission protocol, MAVLink FTP, the preflight
parameter checks and the autopilot's setup)."""
