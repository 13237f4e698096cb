//! Tests of the indirect strategy on small scenes with fixed seeds.
