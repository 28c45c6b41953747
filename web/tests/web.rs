//! Component tests in a real browser (`wasm-pack test --headless --chrome web`).

use floatball_web::components::{ConnectionIndicator, LanguageSwitch};
use floatball_web::connection::Link;
use floatball_web::i18n::Lang;
use leptos::mount::mount_to;
use leptos::prelude::*;
use leptos::task::tick;
use wasm_bindgen::JsCast;
use wasm_bindgen_test::*;

wasm_bindgen_test_configure!(run_in_browser);

fn fresh_container() -> web_sys::HtmlElement {
    let document = document();
    let container = document.create_element("section").unwrap();
    document.body().unwrap().append_child(&container).unwrap();
    container.unchecked_into()
}

fn element(container: &web_sys::HtmlElement, test_id: &str) -> web_sys::HtmlElement {
    container
        .query_selector(&format!("[data-testid={test_id}]"))
        .unwrap()
        .unwrap_or_else(|| panic!("no element with data-testid={test_id}"))
        .unchecked_into()
}

#[wasm_bindgen_test]
async fn connection_indicator_shows_both_states_in_both_languages() {
    let container = fresh_container();
    let link = RwSignal::new(Link::Disconnected);
    let lang = RwSignal::new(Lang::Zh);
    let _mounted = mount_to(container.clone(), move || {
        view! { <ConnectionIndicator link=link lang=lang /> }
    });
    let indicator = element(&container, "connection");
    assert_eq!(indicator.text_content().as_deref(), Some("未连接"));
    assert_eq!(
        indicator.get_attribute("data-state").as_deref(),
        Some("disconnected")
    );

    link.set(Link::Connected);
    tick().await;
    assert_eq!(indicator.text_content().as_deref(), Some("已连接"));
    assert_eq!(
        indicator.get_attribute("data-state").as_deref(),
        Some("connected")
    );

    lang.set(Lang::En);
    tick().await;
    assert_eq!(indicator.text_content().as_deref(), Some("Connected"));

    link.set(Link::Connecting);
    tick().await;
    assert_eq!(indicator.text_content().as_deref(), Some("Not connected"));
    assert_eq!(
        indicator.get_attribute("data-state").as_deref(),
        Some("connecting")
    );
}

#[wasm_bindgen_test]
async fn language_switch_toggles() {
    let container = fresh_container();
    let lang = RwSignal::new(Lang::Zh);
    let _mounted = mount_to(
        container.clone(),
        move || view! { <LanguageSwitch lang=lang /> },
    );
    let switch = element(&container, "lang");
    assert_eq!(switch.text_content().as_deref(), Some("English"));
    switch.click();
    tick().await;
    assert_eq!(lang.get_untracked(), Lang::En);
    assert_eq!(switch.text_content().as_deref(), Some("中文"));
}
