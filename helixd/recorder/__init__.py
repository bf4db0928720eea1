"""Flight recorder: run directory, flight.csv rows, run summary and the events timeline."""

from helixd.recorder.rows import FlightRow, read_flight_columns, read_flight_csv
from helixd.recorder.rundir import RecorderUnavailable, RunRecorder
from helixd.recorder.summary import Arrival, RunSummary, SummaryBuilder

__all__ = [
    "Arrival",
    "FlightRow",
    "RecorderUnavailable",
    "RunRecorder",
    "RunSummary",
    "SummaryBuilder",
    "read_flight_columns",
    "read_flight_csv",
]
