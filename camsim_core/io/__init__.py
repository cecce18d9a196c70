"""Readers and writers: the original simulator's files, raw output, atomic writes."""
