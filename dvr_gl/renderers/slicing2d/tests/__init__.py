"""The tests of this folder's renderer (collected by pytest from the repository root; not installed)."""
