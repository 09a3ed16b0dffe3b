"""Helpers the test files share: plain functions, constants and reference implementations.

Fixtures live in ``tests/conftest.py``; a test file never imports another test file. ``tests/`` is on
``sys.path`` (pytest inserts the folder of the root ``conftest.py``), so these import as ``support.x``.
"""
