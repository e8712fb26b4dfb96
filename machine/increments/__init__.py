"""A small binary protocol for the IPO's per-period axis increments (docs/increment-protocol.md)."""
