"""Bags, CSV tables and stamp pairing: what the tools read and write."""  # noqa: A005
