"""Factory: a real PostgreSQL server from Debian's packages, started in a temporary folder for the tests
(`bench/postgres_server.py`, shared with the service benchmark): trust authentication on a free loopback
port, no fsync; as root it runs as the `postgres` user through `runuser`. Each test gets its own database
(`CREATE DATABASE`), so tests never see each other's rows. `PostgresUnavailable` says why a server could
not be had; the fixtures turn it into a skip with that reason.
"""

from __future__ import annotations

from bench.postgres_server import PostgresServer, PostgresUnavailable, find_bin_dir

__all__ = ["PostgresServer", "PostgresUnavailable", "find_bin_dir"]
