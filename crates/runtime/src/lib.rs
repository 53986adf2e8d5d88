//! The iceoryx2 runtime.
