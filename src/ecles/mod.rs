//! ecles
