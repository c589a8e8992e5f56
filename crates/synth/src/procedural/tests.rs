//! Tests of the default building.
