//! Controller trees (in progress).
