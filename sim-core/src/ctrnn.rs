//! CTRNN (in progress).
