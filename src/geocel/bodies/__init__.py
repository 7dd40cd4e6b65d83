"""Lagrangian bodies of the CEL model (the pile): beams, solids, rigid bodies (DESIGN.md §4.4)."""
