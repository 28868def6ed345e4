//! Feeding the preview renderer: what changed since the last frame goes to the GPU.

use super::{ObjectKey, PreviewState};
use crate::preview::PreviewObject;
use crate::scene::Object;
use crate::worker::Snapshot;
use std::sync::Arc;

impl PreviewState {
    /// The object the preview draws: the chosen one, loaded once, or the painted view's.
    pub(super) fn preview_object(
        &mut self,
        view: Option<(u32, &str, &Arc<Object>)>,
    ) -> Result<Option<(ObjectKey, Arc<Object>)>, String> {
        if self.object == PreviewObject::PaintedView {
            return Ok(view
                .map(|(id, name, object)| (ObjectKey::View(id, name.to_owned()), object.clone())));
        }
        if self.loaded_object.as_ref().map(|(o, _)| o) != Some(&self.object) {
            let object = self.object.load().map_err(|e| e.to_string())?;
            let object = object.expect("a chosen object is not the painted view's");
            self.loaded_object = Some((self.object.clone(), Arc::new(object)));
        }
        let (choice, object) = self.loaded_object.as_ref().expect("loaded above");
        Ok(Some((ObjectKey::Chosen(choice.clone()), object.clone())))
    }

    /// Hands the renderer what changed since the last frame: basis, coefficients, object,
    /// environment, reference table, sparse bins. Small writes only, except when the basis,
    /// a reference or an environment is new.
    pub(super) fn feed(
        &mut self,
        snapshot: &Snapshot,
        view: Option<(u32, &str, &Arc<Object>)>,
    ) -> Option<String> {
        self.render_state.as_ref()?;
        let object = match self.preview_object(view) {
            Ok(object) => object,
            Err(e) => {
                // Back to the painted view's object; the error says why.
                self.object = PreviewObject::PaintedView;
                return Some(format!("preview object: {e}"));
            }
        };
        let rs = self.render_state.as_ref()?;
        let sparse = std::mem::take(&mut self.pending_sparse);
        let basis_changed = match (&snapshot.basis, &self.uploaded_basis) {
            (Some(b), Some(u)) => !Arc::ptr_eq(b, u),
            (Some(_), None) => true,
            _ => false,
        };
        let coefficients_changed = basis_changed || self.uploaded_version != Some(snapshot.version);
        let object_changed = object
            .as_ref()
            .is_some_and(|(key, _)| self.uploaded_object.as_ref() != Some(key));
        let environment_changed = self
            .uploaded_environment
            .as_ref()
            .is_none_or(|e| !Arc::ptr_eq(e, &self.environment));
        let reference = self.reference.as_ref().map(|r| r.table.clone());
        let reference_changed = match (&reference, &self.uploaded_reference) {
            (Some(r), Some(u)) => !Arc::ptr_eq(r, u),
            (Some(_), None) => true,
            _ => false,
        };
        let environment = self.environment.clone();
        let result = crate::preview::with_renderer(
            rs,
            |renderer| -> Result<(), crate::preview::PreviewError> {
                if let (true, Some(basis)) = (basis_changed, &snapshot.basis) {
                    renderer.set_basis(basis)?;
                }
                if coefficients_changed && snapshot.basis.is_some() {
                    renderer.set_coefficients(&snapshot.coefficients)?;
                    renderer.set_fitted_reference(snapshot.reference.as_ref())?;
                }
                if let (true, Some((_, object))) = (object_changed, &object) {
                    renderer.set_object(object)?;
                }
                if environment_changed {
                    renderer.set_environment(&environment);
                }
                if let (true, Some(table)) = (reference_changed, &reference) {
                    renderer.set_table(table)?;
                }
                if !sparse.is_empty() {
                    renderer.update_sparse(&sparse)?;
                }
                Ok(())
            },
        )?;
        if basis_changed {
            self.uploaded_basis = snapshot.basis.clone();
        }
        if coefficients_changed {
            self.uploaded_version = Some(snapshot.version);
        }
        if let (true, Some((key, _))) = (object_changed, object) {
            self.uploaded_object = Some(key);
        }
        if environment_changed {
            self.uploaded_environment = Some(environment);
        }
        if reference_changed {
            self.uploaded_reference = reference;
        }
        result.err().map(|e| e.to_string())
    }
}
