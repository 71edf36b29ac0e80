"""The installed jaxroll's version, for any module that records it (infrastructure: importing it imports nothing
else of jaxroll)."""

import importlib.metadata

try:
    __version__ = importlib.metadata.version("jaxroll")
except importlib.metadata.PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"
