//! The payloads that cross a process boundary.
