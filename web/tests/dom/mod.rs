//! DOM helpers shared by the browser test files: a fresh container to mount into,
//! elements found by their `data-testid`, and waiting on the browser's clock.

// Each test file uses its own subset of these.
#![allow(dead_code)]

use leptos::prelude::{document, window};
use leptos::task::tick;
use wasm_bindgen::JsCast;
use wasm_bindgen_futures::JsFuture;

/// A new empty element at the end of the page's body, for one test to mount into.
pub fn fresh_container() -> web_sys::HtmlElement {
    let document = document();
    let container = document.create_element("section").unwrap();
    document.body().unwrap().append_child(&container).unwrap();
    container.unchecked_into()
}

/// A canvas of `width` × `height` CSS pixels in a fresh container, for a stage.
pub fn fresh_canvas(width: u32, height: u32) -> web_sys::HtmlCanvasElement {
    let canvas: web_sys::HtmlCanvasElement = document()
        .create_element("canvas")
        .unwrap()
        .unchecked_into();
    canvas
        .set_attribute("style", &format!("width: {width}px; height: {height}px"))
        .unwrap();
    fresh_container().append_child(&canvas).unwrap();
    canvas
}

/// Every element in `container` with `data-testid=test_id`, in document order.
pub fn all(container: &web_sys::HtmlElement, test_id: &str) -> Vec<web_sys::HtmlElement> {
    let list = container
        .query_selector_all(&format!("[data-testid={test_id}]"))
        .unwrap();
    (0..list.length())
        .filter_map(|i| list.get(i))
        .map(JsCast::unchecked_into)
        .collect()
}

/// The first element with `data-testid=test_id`; panics naming it if there is none.
pub fn element(container: &web_sys::HtmlElement, test_id: &str) -> web_sys::HtmlElement {
    all(container, test_id)
        .into_iter()
        .next()
        .unwrap_or_else(|| panic!("no element with data-testid={test_id}"))
}

/// The text of the element with `data-testid=test_id`.
pub fn text(container: &web_sys::HtmlElement, test_id: &str) -> String {
    element(container, test_id)
        .text_content()
        .unwrap_or_default()
}

/// An attribute of the element with `data-testid=test_id` ("" when it is missing).
pub fn attribute(container: &web_sys::HtmlElement, test_id: &str, name: &str) -> String {
    element(container, test_id)
        .get_attribute(name)
        .unwrap_or_default()
}

/// Lets `ms` of the browser's time pass.
pub async fn sleep(ms: i32) {
    let promise = js_sys::Promise::new(&mut |resolve, _| {
        window()
            .set_timeout_with_callback_and_timeout_and_arguments_0(&resolve, ms)
            .unwrap();
    });
    JsFuture::from(promise).await.unwrap();
}

/// Waits (up to `within_ms`) until `condition` holds; panics naming `what` if not.
pub async fn until_within(what: &str, within_ms: i32, condition: impl Fn() -> bool) {
    for _ in 0..within_ms / 10 {
        tick().await;
        if condition() {
            return;
        }
        sleep(10).await;
    }
    panic!("timed out waiting until {what}");
}

/// Waits (up to 3 s) until `condition` holds.
pub async fn until(what: &str, condition: impl Fn() -> bool) {
    until_within(what, 3000, condition).await;
}

/// Sets an input's, a textarea's or a select's value and sends the event a user's
/// change would.
pub fn set_value(container: &web_sys::HtmlElement, test_id: &str, value: &str, event: &str) {
    let field = element(container, test_id);
    if let Some(input) = field.dyn_ref::<web_sys::HtmlInputElement>() {
        input.set_value(value);
    } else if let Some(text) = field.dyn_ref::<web_sys::HtmlTextAreaElement>() {
        text.set_value(value);
    } else {
        field
            .unchecked_ref::<web_sys::HtmlSelectElement>()
            .set_value(value);
    }
    let init = web_sys::EventInit::new();
    init.set_bubbles(true);
    let event = web_sys::Event::new_with_event_init_dict(event, &init).unwrap();
    field.dispatch_event(&event).unwrap();
}
