//! Jog accuracy tests against an independent analytic model.
