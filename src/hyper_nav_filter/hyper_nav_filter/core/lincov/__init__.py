"""Linear covariance analysis (LinCov) of the configured filter: the true
estimation-error covariance along a reference trajectory against the
truth's own error models, and its split by error source.

  linear  the generic suboptimal-filter covariance recursion, by input group
  truth   the world's error sources as data (augmented states, white noises)
  ins     the INS filter's matrices from its state blocks and measurement models
"""
from .ins import INIT_GROUPS, InsLinCov, LinCovResult, LooseGnss, Reference
from .linear import LinCov
from .truth import TruthModel, TruthSource

__all__ = ["LinCov", "TruthModel", "TruthSource", "InsLinCov", "LinCovResult", "LooseGnss", "Reference",
           "INIT_GROUPS"]
