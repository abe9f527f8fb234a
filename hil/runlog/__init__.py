"""The run log: the MCAP writer, reading and recovering run logs, and the completeness account of a
recording."""
