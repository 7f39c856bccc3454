export const PROTOCOL_MAJOR: 1;
export const CATALOGUE_MINOR: 15;
export const PARTS: Readonly<{
    ChannelInfo: string[][];
}>;
export const CODES: readonly {
    name: string;
    code: number;
    minor: number;
    direction: string;
    via: string;
    family: string;
    body: string[][];
    reply: string[][];
}[];
export const ERRORS: readonly (string | number)[][];
export const CHANNEL_KINDS: readonly (string | number)[][];
