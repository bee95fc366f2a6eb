//! The nomen recording format: a validating streaming JSON Lines reader and writer, plus CSV import.
