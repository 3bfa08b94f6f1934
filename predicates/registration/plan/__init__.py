"""Everything decided before the registration proper (the paper's section 1 premises):
the call's inputs and their validation, exact power-of-two scaling, the refinement of
coarse cutting meshes, L over the cells that can meet and the resolution report
(docs/resolution.md), and the threads the plan's per-cell passes run on."""
