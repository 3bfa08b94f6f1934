"""Spatial search shared by every stage: blocks of rows (bounded memory), exact bounding
boxes, the broad phase's top grid and summed-area tables, and boxes within a distance by
grid hashing (docs/design.md, "Broad phase")."""
