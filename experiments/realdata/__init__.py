"""Real UR5e demonstrations through the product: contact events against hand labels, the guiding hand's
force against the contact reaction, and reproductions played from each demonstration's first frame
(``python -m experiments.realdata``; writes ``results/realdata.md``)."""
