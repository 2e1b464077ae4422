"""flexmb's version (one place: the package, the database files and the command line read it)."""

__version__ = "0.1.0"
