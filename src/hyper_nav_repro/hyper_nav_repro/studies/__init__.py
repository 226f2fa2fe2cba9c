"""Design studies on a user's vehicle (issue 39): LinCov error budgets, grade sweeps, LinCov vs Monte Carlo."""
