//! The Create page's planner worker in a real browser (`wasm-pack test --headless
//! --chrome web --test browser -- plan_worker::`): with no app module named in the page none is
//! started; one whose script cannot run (this test server has no
//! `/plan-worker.js`) answers the pending request with the failure and takes no more
//! work, so the page plans on its own thread instead. The worker at work — the
//! verdict planned off the page's thread — is the end-to-end test
//! `a_newcomer_makes_a_show_on_the_phone_and_plays_it_on_the_matrix`.

use std::cell::RefCell;
use std::rc::Rc;

use floatball_web::plan_worker::{Answer, PlanWorker};
use wasm_bindgen_test::*;

use crate::dom::*;

#[wasm_bindgen_test]
async fn a_worker_that_cannot_run_says_so_and_takes_no_more_work() {
    assert!(
        PlanWorker::start(|_, _| {}).is_none(),
        "no app module in the page: no worker"
    );
    let document = web_sys::window().unwrap().document().unwrap();
    let link = document.create_element("link").unwrap();
    link.set_attribute("rel", "modulepreload").unwrap();
    link.set_attribute("href", "/no-such-app.js").unwrap();
    document.head().unwrap().append_child(&link).unwrap();

    let answers: Rc<RefCell<Vec<(u32, Answer)>>> = Rc::default();
    let worker = {
        let answers = Rc::clone(&answers);
        PlanWorker::start(move |id, answer| answers.borrow_mut().push((id, answer)))
    }
    .expect("a module worker");
    assert!(worker.plan(7, "{}", "{}"));
    for _ in 0..300 {
        if !answers.borrow().is_empty() {
            break;
        }
        sleep(10).await;
    }
    assert!(
        !answers.borrow().is_empty(),
        "the failure is heard within 3 s"
    );
    let (id, answer) = answers.borrow_mut().remove(0);
    assert_eq!(id, 7);
    let error = answer.expect_err("a worker without its script fails");
    assert!(error.contains("/plan-worker.js"), "{error}");
    assert!(
        !worker.plan(8, "{}", "{}"),
        "a failed worker takes no more work"
    );
    drop(worker);
    link.remove();
}
