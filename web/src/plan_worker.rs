//! The Create page's planner in a Web Worker (`static/plan-worker.js`), so that
//! planning a large show never holds the page's thread: at 100 × 100 balls for a
//! minute the plan takes about a second, during which no button — the E-STOP
//! included — would answer.
//!
//! The worker loads the app's own module (the page's `modulepreload` link) and runs
//! [`crate::create::plan_recipe`] on the recipe and the installation, as JSON: the
//! same code the page would run, so the same verdict. Where no worker can be made
//! (no built app in the page, as in the browser tests), [`PlanWorker::start`] gives
//! `None` and the page plans on its own thread as before.

use std::cell::{Cell, RefCell};
use std::rc::Rc;

use floatball_shared::api::PlanReport;
use wasm_bindgen::JsCast;
use wasm_bindgen::prelude::{Closure, JsValue};
use web_sys::{MessageEvent, Worker, WorkerOptions, WorkerType};

/// Where the worker's script is served.
pub const SCRIPT: &str = "/plan-worker.js";

/// What the worker answers for a request: the verdict (none offline), or why it
/// could not plan.
pub type Answer = Result<Option<PlanReport>, String>;

/// A running planner worker; terminated when dropped.
pub struct PlanWorker {
    worker: Worker,
    module: String,
    /// The last request's id, and whether the worker has failed (then [`Self::plan`]
    /// refuses, and the page plans on its own thread).
    pending: Rc<Cell<u32>>,
    failed: Rc<Cell<bool>>,
    _on_message: Closure<dyn FnMut(MessageEvent)>,
    _on_error: Closure<dyn FnMut(web_sys::Event)>,
}

impl PlanWorker {
    /// Starts the worker; `on_answer(id, answer)` is called for every answer, and
    /// with an error for the pending request if the worker itself fails (its script
    /// missing, its module refused). `None` when the page names no app module or the
    /// browser makes no module worker.
    pub fn start(on_answer: impl FnMut(u32, Answer) + 'static) -> Option<Self> {
        let document = web_sys::window()?.document()?;
        let link = document
            .query_selector("link[rel=modulepreload]")
            .ok()
            .flatten()?;
        let href = link.get_attribute("href")?;
        let module = web_sys::Url::new_with_base(&href, &document.url().ok()?)
            .ok()?
            .href();
        let options = WorkerOptions::new();
        options.set_type(WorkerType::Module);
        let worker = Worker::new_with_options(SCRIPT, &options).ok()?;
        let on_answer = Rc::new(RefCell::new(on_answer));
        let pending = Rc::new(Cell::new(0));
        let failed = Rc::new(Cell::new(false));
        let on_message = {
            let (on_answer, failed) = (Rc::clone(&on_answer), Rc::clone(&failed));
            Closure::<dyn FnMut(MessageEvent)>::new(move |event: MessageEvent| {
                let data = event.data();
                let field = |name: &str| js_sys::Reflect::get(&data, &JsValue::from_str(name)).ok();
                let id = field("id").and_then(|id| id.as_f64()).unwrap_or(-1.0);
                let Ok(id) = u32::try_from(id as i64) else {
                    return;
                };
                let answer = match field("report").and_then(|report| report.as_string()) {
                    Some(report) => serde_json::from_str::<Option<PlanReport>>(&report)
                        .map_err(|error| format!("the worker's verdict cannot be read: {error}")),
                    None => Err(field("error")
                        .and_then(|error| error.as_string())
                        .unwrap_or_else(|| "the planner worker failed".to_owned())),
                };
                if answer.is_err() {
                    failed.set(true);
                }
                if let Ok(mut on_answer) = on_answer.try_borrow_mut() {
                    on_answer(id, answer);
                }
            })
        };
        let on_error = {
            let (pending, failed) = (Rc::clone(&pending), Rc::clone(&failed));
            Closure::<dyn FnMut(web_sys::Event)>::new(move |event: web_sys::Event| {
                event.prevent_default();
                failed.set(true);
                if let Ok(mut on_answer) = on_answer.try_borrow_mut() {
                    on_answer(
                        pending.get(),
                        Err(format!("the planner worker ({SCRIPT}) could not run")),
                    );
                }
            })
        };
        worker.set_onmessage(Some(on_message.as_ref().unchecked_ref()));
        worker.set_onerror(Some(on_error.as_ref().unchecked_ref()));
        Some(Self {
            worker,
            module,
            pending,
            failed,
            _on_message: on_message,
            _on_error: on_error,
        })
    }

    /// Asks for the verdict on `recipe_json` for `installation_json`, answered with
    /// `id`. `false` if the worker has failed or the request could not be sent.
    pub fn plan(&self, id: u32, recipe_json: &str, installation_json: &str) -> bool {
        if self.failed.get() {
            return false;
        }
        let message = js_sys::Object::new();
        let set = |name: &str, value: JsValue| {
            js_sys::Reflect::set(&message, &JsValue::from_str(name), &value).is_ok()
        };
        self.pending.set(id);
        set("module", JsValue::from_str(&self.module))
            && set("id", JsValue::from(id))
            && set("recipe", JsValue::from_str(recipe_json))
            && set("installation", JsValue::from_str(installation_json))
            && self.worker.post_message(&message).is_ok()
    }
}

impl std::fmt::Debug for PlanWorker {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PlanWorker")
            .field("module", &self.module)
            .finish_non_exhaustive()
    }
}

impl Drop for PlanWorker {
    fn drop(&mut self) {
        self.worker.terminate();
    }
}
