//! The background worker: changed pixels in, immutable solution snapshots out.
