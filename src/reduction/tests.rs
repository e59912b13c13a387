//! Integration tests of the reduction methods against the full model.
