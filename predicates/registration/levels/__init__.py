"""The registration proper: rank-space complexes of the cells that can meet, every kind's
candidate face pairs, and the level loop with suppression by registered sub-pairs
(section 1 of the paper; Algorithms 2–5 and 7–12 evaluated in numpy batch mode)."""
