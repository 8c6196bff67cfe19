"""Acquisition: plans (generators of small commands) and the engine that runs them on
real or simulated devices, emitting the documents of :mod:`labjoint.documents` (which
storage subscribes to).
"""
