"""Seed 003 (Chen et al. 2020, geomagnetic aided navigation) reproduction."""
