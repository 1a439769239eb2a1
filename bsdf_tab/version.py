"""The package version (one place; every module that records it imports it from here)."""

__version__ = "0.3.3"
