//! Sensor models (in progress).
