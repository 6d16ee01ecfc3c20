"""The package version, in a module of its own: the package root, the command line and the FOLD
writer read it without importing one another."""

__version__ = "0.1.0"
