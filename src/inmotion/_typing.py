"""Type aliases of the public API."""
from __future__ import annotations

import os
from typing import Union

__all__ = ["PathLike"]

#: a file or folder: ``str`` or ``pathlib.Path`` (anything ``os.fspath`` takes)
PathLike = Union[str, "os.PathLike[str]"]
