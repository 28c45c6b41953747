//! The password form's fixed strings, in both languages: the form is shown in
//! Settings and, once per installation, as the forced change at the first login,
//! both in chunks of their own, so its strings come with them.

texts! {
    /// The password form's fixed strings (Settings and the forced change at the first login): they come with its chunk.
    PasswordText;
    /// The forced password change: title.
    ChangePasswordTitle => "请修改初始密码", "Change the factory password";
    /// The forced password change: why.
    ChangePasswordNote => "初始密码必须修改后才能上传文件和控制浮球。", "The factory password must be changed before files can be uploaded or the matrix controlled.";
    /// Label: the current password (when the app does not have it).
    CurrentPassword => "当前密码", "Current password";
    /// Label: the new password.
    NewPassword => "新密码", "New password";
    /// Label: the new password again.
    ConfirmPassword => "确认新密码", "Confirm the new password";
    /// The change-password button.
    ChangePasswordButton => "修改密码", "Change password";
    /// The two new passwords differ.
    PasswordsDiffer => "两次输入的新密码不一致", "The two new passwords differ";
    /// 401 on a password change.
    WrongCurrentPassword => "当前密码错误", "The current password is wrong";
    /// The password was changed.
    PasswordChanged => "密码已修改", "The password was changed";
    /// Settings: what a password change does to other logins.
    PasswordChangeNote => "修改后，其他设备上的登录将失效，需要用新密码重新登录。", "Logins on other devices end; they log in again with the new password.";
}
