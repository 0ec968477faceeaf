"""nudge: simulate and analyse assistive shared-control studies.

The model of *Information Theoretic Intent Disambiguation via Contextual Nudges for
Assistive Shared Control*: interface-aware goal inference for a sip-and-puff driven
3-DoF robot, the disambiguation metric D(s), turn taking with linear blending, simulated
participants, the paper's metrics, statistics and figures.
"""

__version__ = "0.1.0"
