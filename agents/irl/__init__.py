"""Learning the humans' costs by inverse optimal control.

Continuous IRL with the Laplace approximation (laplace, with exact derivatives from jets),
discrete-choice IRL on recorded decisions (choice), and near-rational synthetic demonstrations
(synthetic).
"""
