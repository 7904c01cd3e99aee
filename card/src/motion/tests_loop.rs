//! Closed-loop and safety tests with a plant model.
