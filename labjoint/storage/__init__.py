"""Storage: NeXus-style HDF5 run files, the SQLite catalog, CSV import.

The run writer subscribes to the documents acquisition emits; the reader returns
physical units (:class:`labjoint.storage.run.Run`).
"""
