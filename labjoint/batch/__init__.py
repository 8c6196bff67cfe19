"""Batch work over a lab's archive: reprocess runs and sweep models, serially or on Dask.

:func:`~labjoint.batch.reprocess.plan_reprocess` and
:func:`~labjoint.batch.reprocess.execute` are the engine-agnostic part;
:mod:`labjoint.batch.cluster` runs the tasks on a Dask LocalCluster or scheduler.
"""
