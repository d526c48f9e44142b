"""Success-verified simulation augmentation (paper A.7): perturb, re-simulate, judge, render, write."""
