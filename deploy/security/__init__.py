"""Locking a LunarSim keyspace down: TLS with mutual authentication, user/password auth, access control."""
