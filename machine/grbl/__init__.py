"""Streaming to grbl 1.1 boards: protocol facts, what is streamed, the ledger and the serial link."""
