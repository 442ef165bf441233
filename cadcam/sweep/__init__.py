"""Parameter studies: study files and sweeps recorded to SQLite."""
