// TalkingHead (@met4citizen/talkinghead), an entry of its own so that the build puts it in
// ../static/vendor/ beside three.js's core, with the files it loads beside it at run time (its
// playback worklet and its English lip-sync module).
export { TalkingHead } from "@met4citizen/talkinghead";
