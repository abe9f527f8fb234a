"""Shipped hydrodynamic data (npz); sources and conversion in this folder's README.md."""
