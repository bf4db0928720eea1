"""The file names of a run directory, declared once: the recorder writes them, the readers
(replay, plot, export, resume) and the inputs record of ``--resume`` name them."""

from __future__ import annotations

FLIGHT_FILE = "flight.csv"  # one row per control step (helixd.recorder.rows)
SUMMARY_FILE = "summary.json"  # helixd.recorder.summary.RunSummary
EVENTS_FILE = "events.jsonl"  # every structlog event of the run
CONFIG_FILE = "config.yaml"  # the config as flown
MISSION_FILE = "mission.yaml"  # the mission as flown (what --resume re-reads and hashes)
INPUTS_FILE = "inputs.json"  # helixd.mission.resume.RunInputs (mission/config hashes)
TLOG_FILE = "link.tlog"  # every MAVLink frame of the link (helixd.link.wire.tlog, link.tlog_*)
PAYLOAD_FILE = "payload.csv"  # the sensors' readings where taken (helixd.recorder.payload_log)
