//! Tests of program statement parsing and listing round trips.
