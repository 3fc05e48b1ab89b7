"""Ingest: read a log (the recording format or an authors' native format), check it, and find
its releases.  Nothing here fits or simulates."""
