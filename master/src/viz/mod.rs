//! Pictures of what evolved (in progress).
