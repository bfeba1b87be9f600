"""Readers and writers: the only place (with report/) where pandas and pyarrow are used."""
