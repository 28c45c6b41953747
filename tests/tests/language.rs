//! One language everywhere, as a user meets it: the app opens in the browser's
//! language (中文 for `zh…`, English otherwise) unless the operator chose one before,
//! `<html lang>` follows every switch, and the bridge's refusals (a password it
//! refuses, a CSV file it cannot import) read in 中文 in a 中文 app.

use floatball_e2e::{Bridge, Browser, INDICATOR, UI_TIMEOUT};

#[tokio::test]
async fn the_app_opens_in_the_browsers_language_and_html_lang_follows_the_switch() {
    let bridge = Bridge::start().await;

    let english = Browser::open_in(&bridge, "en-US").await;
    english
        .wait_for_attribute(INDICATOR, "data-state", "disconnected", UI_TIMEOUT)
        .await;
    english.wait_for_text("[data-testid=lang]", "中文").await;
    assert_eq!(english.text(INDICATOR).await, "Not connected");
    assert_eq!(english.document_lang().await, "en");

    // The switch changes the texts and <html lang>, and is remembered: a reload
    // stays in the chosen language although the browser's is English.
    english.click("[data-testid=lang]").await;
    english.wait_for_text(INDICATOR, "未连接").await;
    assert_eq!(english.document_lang().await, "zh");
    english.client.refresh().await.expect("reload");
    english.wait_for_text(INDICATOR, "未连接").await;
    assert_eq!(english.document_lang().await, "zh");
    english.click("[data-testid=lang]").await;
    english.wait_for_text(INDICATOR, "Not connected").await;
    assert_eq!(english.document_lang().await, "en");
    english.client.close().await.expect("close the browser");

    let chinese = Browser::open_in(&bridge, "zh-CN").await;
    chinese.wait_for_text(INDICATOR, "未连接").await;
    assert_eq!(chinese.document_lang().await, "zh");
    chinese.client.close().await.expect("close the browser");
}

#[tokio::test]
async fn the_bridges_refusals_read_in_chinese() {
    let bridge = Bridge::start().await;
    let browser = Browser::open_in(&bridge, "zh-CN").await;

    // The bridge refuses a new password that is too short: its code, in 中文.
    browser.log_in("1234").await;
    browser.wait_for("[data-testid=password-form]").await;
    browser.type_into("[data-testid=password-new]", "abc").await;
    browser
        .type_into("[data-testid=password-confirm]", "abc")
        .await;
    browser.click("[data-testid=password-submit]").await;
    browser
        .wait_for_text("[data-testid=password-error]", "新密码太短：至少 4 个字符")
        .await;

    // A CSV the bridge cannot import: the problem, with its line and column, in 中文.
    browser
        .type_into("[data-testid=password-new]", "night-show-7")
        .await;
    browser
        .type_into("[data-testid=password-confirm]", "night-show-7")
        .await;
    browser.click("[data-testid=password-submit]").await;
    browser.wait_for("[data-testid=page-files]").await;
    let folder = tempfile::tempdir().expect("temp dir");
    let path = folder.path().join("bad.csv");
    std::fs::write(&path, "# rows=1 cols=1\ntime_ms,u0\n0,0\n50,x\n").expect("write the CSV");
    browser.pick_file("[data-testid=file-picker]", &path).await;
    browser
        .wait_for("[data-testid=local-file][data-name='bad.csv']")
        .await;
    browser.click("[data-testid=upload]").await;
    browser
        .wait_for_text("[data-testid=files-message]", "无法导入这个 CSV 关键帧文件")
        .await;
    browser
        .wait_for_text(
            "[data-testid=upload-details]",
            "第 4 行第 2 列：“x”不是数字",
        )
        .await;
    let message = browser.text("[data-testid=files-message]").await;
    assert!(!message.contains("not a number"), "{message}");
    browser.client.close().await.expect("close the browser");
}
