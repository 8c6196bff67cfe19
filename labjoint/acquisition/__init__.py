"""Acquisition: plans (generators of small commands), the engine that runs them on
real or simulated devices, and the documents a run emits (which storage subscribes to).
"""
