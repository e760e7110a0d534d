//! Client library for cliffd (under construction).
