"""MCAP field logs: writing, reading, checking and recovering (see docs/logs.md)."""
