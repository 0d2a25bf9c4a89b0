"""``python -m inmotion ...``: the command line (:mod:`inmotion.cli.main`)."""
from inmotion.cli.main import entry

entry()
