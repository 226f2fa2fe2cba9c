"""Seed 004 (Gao et al. 2023, virtual GNSS under lock loss) reproduction."""
