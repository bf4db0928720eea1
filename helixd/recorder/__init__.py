"""Flight recorder: run directory, flight.csv rows, run summary and the events timeline."""
