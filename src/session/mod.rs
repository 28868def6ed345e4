//! Session files: every view's scene and painting, brush and basis settings, in one file; autosave and recovery.
