"""Storage: NeXus-style HDF5 run files, the catalog (SQLite or PostgreSQL), CSV import.

The run writer subscribes to the documents acquisition emits; the reader returns
physical units (:class:`labjoint.storage.run.Run`).
"""

from labjoint.storage.catalog import Catalog, RunRecord, catalog_for, open_catalog
from labjoint.storage.csv_import import import_csv
from labjoint.storage.processed import read_processed, write_processed
from labjoint.storage.reader import DataBlock, RunFile, is_csv, open_run, read_any, read_run
from labjoint.storage.recover import recover, recover_all
from labjoint.storage.run import Run
from labjoint.storage.writer import RunWriter

__all__ = ["Catalog", "RunRecord", "catalog_for", "open_catalog", "import_csv", "read_processed", "write_processed",
           "DataBlock", "RunFile", "is_csv", "open_run", "read_any", "read_run", "recover", "recover_all", "Run",
           "RunWriter"]
