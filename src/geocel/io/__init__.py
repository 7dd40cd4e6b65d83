"""Run outputs: the history table, field snapshots for ParaView, checkpoints and the run directory.

Every writer leaves a readable file when the process is killed: the history is appended line by line
with single writes, and whole files (``.pvd``, checkpoints, ``summary.json``, ``config.toml``) are
written to a temporary file and moved into place with ``os.replace``.
"""
