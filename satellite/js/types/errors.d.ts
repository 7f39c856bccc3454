/**
 * The error for a wire error value (u16) and the hub's message.
 * @param {number} value
 * @param {string} message
 * @returns {FlowError}
 */
export function errorFromWire(value: number, message: string): FlowError;
/** The wire value of each error name, from the catalogue. @type {Readonly<Record<string, number>>} */
export const ERROR_VALUES: Readonly<Record<string, number>>;
/** A failure reported by the hub (or by the library on its behalf). */
export class FlowError extends Error {
    /**
     * @param {string} code the catalogue's error name ("not_found"), or "closed"
     * @param {string} message
     */
    constructor(code: string, message: string);
    /** @type {string} */
    code: string;
}
/** `protocol_error` */
export class ProtocolError extends FlowError {
    /** @param {string} message */
    constructor(message: string);
}
/** `version_mismatch` */
export class VersionMismatchError extends FlowError {
    /** @param {string} message */
    constructor(message: string);
}
/** `auth_failed` */
export class AuthFailedError extends FlowError {
    /** @param {string} message */
    constructor(message: string);
}
/** `not_logged_in` */
export class NotLoggedInError extends FlowError {
    /** @param {string} message */
    constructor(message: string);
}
/** `not_found` */
export class NotFoundError extends FlowError {
    /** @param {string} message */
    constructor(message: string);
}
/** `already_exists` */
export class AlreadyExistsError extends FlowError {
    /** @param {string} message */
    constructor(message: string);
}
/** `permission_denied` */
export class PermissionDeniedError extends FlowError {
    /** @param {string} message */
    constructor(message: string);
}
/** `invalid_argument` */
export class InvalidArgumentError extends FlowError {
    /** @param {string} message */
    constructor(message: string);
}
/** `timeout` */
export class TimeoutError extends FlowError {
    /** @param {string} message */
    constructor(message: string);
}
/** `owner_gone` */
export class OwnerGoneError extends FlowError {
    /** @param {string} message */
    constructor(message: string);
}
/** `overflow` */
export class OverflowError extends FlowError {
    /** @param {string} message */
    constructor(message: string);
}
/** `unsupported` */
export class UnsupportedError extends FlowError {
    /** @param {string} message */
    constructor(message: string);
}
/** `limit_exceeded` */
export class LimitExceededError extends FlowError {
    /** @param {string} message */
    constructor(message: string);
}
/** `io_error` */
export class IoError extends FlowError {
    /** @param {string} message */
    constructor(message: string);
}
/** `internal` */
export class InternalError extends FlowError {
    /** @param {string} message */
    constructor(message: string);
}
/** The connection closed before the answer came (`closed`; never on the wire). */
export class ClosedError extends FlowError {
    /** @param {string} message */
    constructor(message: string);
}
/** The subclass of each error name (ok has none). */
export const ERROR_CLASSES: Readonly<{
    protocol_error: typeof ProtocolError;
    version_mismatch: typeof VersionMismatchError;
    auth_failed: typeof AuthFailedError;
    not_logged_in: typeof NotLoggedInError;
    not_found: typeof NotFoundError;
    already_exists: typeof AlreadyExistsError;
    permission_denied: typeof PermissionDeniedError;
    invalid_argument: typeof InvalidArgumentError;
    timeout: typeof TimeoutError;
    owner_gone: typeof OwnerGoneError;
    overflow: typeof OverflowError;
    unsupported: typeof UnsupportedError;
    limit_exceeded: typeof LimitExceededError;
    io_error: typeof IoError;
    internal: typeof InternalError;
}>;
