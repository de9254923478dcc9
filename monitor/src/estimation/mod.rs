//! Estimation: the six-state model and its Jacobian, the EKF core, the
//! bank of one filter per leak hypothesis, the innovation-consistency
//! check and the quiet-period detector.

pub(crate) mod bank;
pub(crate) mod consistency;
pub(crate) mod ekf;
pub(crate) mod model;
pub(crate) mod quiet;
