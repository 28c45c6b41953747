//! Local show files in the browser's IndexedDB, so they survive reloads and restarts
//! of the browser (localStorage would cap them at a few MB and block the page while
//! writing).
//!
//! One object store, `files`, keyed by file name; each value is a [`LocalFile`] as
//! JSON text.

use wasm_bindgen::closure::Closure;
use wasm_bindgen::{JsCast, JsValue};
use wasm_bindgen_futures::JsFuture;
use web_sys::{IdbDatabase, IdbOpenDbRequest, IdbRequest, IdbTransactionMode};

use crate::files::LocalFile;
use crate::http::describe_js_error;

/// The object store's name.
const STORE: &str = "files";
/// The database schema's version.
const VERSION: u32 = 1;

/// The app's database of local files.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LocalStore {
    database: String,
}

impl Default for LocalStore {
    fn default() -> Self {
        Self::new("floatball")
    }
}

impl LocalStore {
    /// The store in the IndexedDB database `database` (tests use their own).
    pub fn new(database: &str) -> Self {
        Self {
            database: database.to_owned(),
        }
    }

    async fn open(&self) -> Result<IdbDatabase, String> {
        let factory = web_sys::window()
            .ok_or("no window")?
            .indexed_db()
            .map_err(describe_js_error)?
            .ok_or("IndexedDB is not available in this browser")?;
        let request: IdbOpenDbRequest = factory
            .open_with_u32(&self.database, VERSION)
            .map_err(describe_js_error)?;
        let upgrade = Closure::<dyn FnMut(web_sys::Event)>::new(|event: web_sys::Event| {
            let database = event
                .target()
                .and_then(|target| target.dyn_into::<IdbRequest>().ok())
                .and_then(|request| request.result().ok())
                .and_then(|result| result.dyn_into::<IdbDatabase>().ok());
            if let Some(database) = database
                && !database.object_store_names().contains(STORE)
                && let Err(error) = database.create_object_store(STORE)
            {
                leptos::logging::warn!(
                    "cannot create the file store: {}",
                    crate::http::describe_js_error(error)
                );
            }
        });
        request.set_onupgradeneeded(Some(upgrade.as_ref().unchecked_ref()));
        let result = finished(&request).await;
        request.set_onupgradeneeded(None);
        drop(upgrade);
        result?
            .dyn_into::<IdbDatabase>()
            .map_err(|_| "IndexedDB did not open".to_owned())
    }

    /// Every stored file (unreadable records are skipped).
    ///
    /// # Errors
    /// The browser's error, as text.
    pub async fn load_all(&self) -> Result<Vec<LocalFile>, String> {
        let database = self.open().await?;
        let store = database
            .transaction_with_str(STORE)
            .and_then(|transaction| transaction.object_store(STORE))
            .map_err(describe_js_error)?;
        let all = finished(&store.get_all().map_err(describe_js_error)?).await?;
        database.close();
        let files = js_sys::Array::from(&all)
            .iter()
            .filter_map(|value| value.as_string())
            .filter_map(|text| serde_json::from_str(&text).ok())
            .collect();
        Ok(files)
    }

    /// Stores `file`, replacing one of the same name.
    ///
    /// # Errors
    /// The browser's error, as text (e.g. the storage quota is full).
    pub async fn put(&self, file: &LocalFile) -> Result<(), String> {
        let text = serde_json::to_string(file).map_err(|err| err.to_string())?;
        self.write(|store| {
            store.put_with_key(&JsValue::from_str(&text), &file.name.as_str().into())
        })
        .await
    }

    /// Deletes the file named `name` (nothing if there is none).
    ///
    /// # Errors
    /// The browser's error, as text.
    pub async fn delete(&self, name: &str) -> Result<(), String> {
        self.write(|store| store.delete(&name.into())).await
    }

    async fn write(
        &self,
        operation: impl FnOnce(&web_sys::IdbObjectStore) -> Result<IdbRequest, JsValue>,
    ) -> Result<(), String> {
        let database = self.open().await?;
        let store = database
            .transaction_with_str_and_mode(STORE, IdbTransactionMode::Readwrite)
            .and_then(|transaction| transaction.object_store(STORE))
            .map_err(describe_js_error)?;
        let request = operation(&store).map_err(describe_js_error)?;
        let result = finished(&request).await;
        database.close();
        result.map(drop)
    }
}

/// Waits for `request` to succeed (its result) or fail (its error, as text).
async fn finished(request: &IdbRequest) -> Result<JsValue, String> {
    let promise = js_sys::Promise::new(&mut |resolve, reject| {
        request.set_onsuccess(Some(&resolve));
        request.set_onerror(Some(&reject));
    });
    let outcome = JsFuture::from(promise).await;
    request.set_onsuccess(None);
    request.set_onerror(None);
    outcome.map_err(|_| match request.error() {
        Ok(Some(error)) => error.message(),
        _ => "IndexedDB request failed".to_owned(),
    })?;
    request.result().map_err(describe_js_error)
}
