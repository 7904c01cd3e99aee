//! Tests of on-line command parsing.
