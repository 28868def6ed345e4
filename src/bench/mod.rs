//! `burnish bench`: run time against error, and the live-loop timings.
