"""Example policies of researchers' own, run by experiment files beside this folder (docs/policies.md)."""
