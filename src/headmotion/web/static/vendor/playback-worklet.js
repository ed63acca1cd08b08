/*! TalkingHead (@met4citizen/talkinghead 1.7.0), https://github.com/met4citizen/TalkingHead
MIT License

Copyright (c) 2023-2024 Mika Suominen

Permission is hereby granted, free of charge, to any person obtaining a copy
of this software and associated documentation files (the "Software"), to deal
in the Software without restriction, including without limitation the rights
to use, copy, modify, merge, publish, distribute, sublicense, and/or sell
copies of the Software, and to permit persons to whom the Software is
furnished to do so, subject to the following conditions:

The above copyright notice and this permission notice shall be included in all
copies or substantial portions of the Software.

THE SOFTWARE IS PROVIDED "AS IS", WITHOUT WARRANTY OF ANY KIND, EXPRESS OR
IMPLIED, INCLUDING BUT NOT LIMITED TO THE WARRANTIES OF MERCHANTABILITY,
FITNESS FOR A PARTICULAR PURPOSE AND NONINFRINGEMENT. IN NO EVENT SHALL THE
AUTHORS OR COPYRIGHT HOLDERS BE LIABLE FOR ANY CLAIM, DAMAGES OR OTHER
LIABILITY, WHETHER IN AN ACTION OF CONTRACT, TORT OR OTHERWISE, ARISING FROM,
OUT OF OR IN CONNECTION WITH THE SOFTWARE OR THE USE OR OTHER DEALINGS IN THE
SOFTWARE.
*/
// built by web/js/build.mjs.
var l=class i extends AudioWorkletProcessor{static FSM={IDLE:0,PLAYING:1};constructor(h){super(),this.port.onmessage=this.handleMessage.bind(this),this._sampleRate=h?.processorOptions?.sampleRate||sampleRate,this._scale=1/32768;let r=1;this._silenceThresholdBlocks=Math.ceil(this._sampleRate*r/128);let e=h?.processorOptions?.metrics||{};this._metricsEnabled=e.enabled!==!1;let t=typeof e.intervalHz=="number"&&e.intervalHz>0?e.intervalHz:2;this._framesProcessed=0,this._underrunBlocks=0,this._maxQueueSamples=0,this._lastMetricsSentAtFrame=0,this._metricsIntervalFrames=Math.max(128,Math.round(this._sampleRate/t)),this.reset()}reset(){this._bufferQueue=[],this._currentChunk=null,this._currentChunkOffset=0,this._state=i.FSM.IDLE,this._noMoreDataReceived=!1,this._silenceFramesCount=0,this._hasSentEnded=!1,this._maxQueueSamples=0}handleMessage(h){let{type:r,data:e}=h.data;if(r==="stop"){if(this.reset(),this._metricsEnabled)try{this.port.postMessage({type:"metrics",data:{state:i.FSM.IDLE,queuedSamples:0,queuedMs:0,maxQueuedMs:Math.round(this._maxQueueSamples/this._sampleRate*1e3),underrunBlocks:this._underrunBlocks,framesProcessed:this._framesProcessed}})}catch{}return}if(r==="no-more-data"){this._noMoreDataReceived=!0;return}if(r==="config-metrics"&&e&&typeof e=="object"){if("enabled"in e&&(this._metricsEnabled=!!e.enabled),typeof e.intervalHz=="number"&&e.intervalHz>0){let t=e.intervalHz;this._metricsIntervalFrames=Math.max(128,Math.round(this._sampleRate/t))}this._lastMetricsSentAtFrame=this._framesProcessed;return}r==="audioData"&&e instanceof ArrayBuffer&&(this._noMoreDataReceived=!1,this._state===i.FSM.IDLE&&(this._state=i.FSM.PLAYING,this.port.postMessage({type:"playback-started"})),this._state===i.FSM.PLAYING&&(this._bufferQueue.push(new Int16Array(e)),this._silenceFramesCount=0))}process(h,r,e){let t=r[0]?.[0];if(!t)return!0;if(this._state!==i.FSM.PLAYING)return t.fill(0),!0;let u=t.length,n=0;for(;n<u;){if(!this._currentChunk||this._currentChunkOffset>=this._currentChunk.length)if(this._bufferQueue.length>0)this._currentChunk=this._bufferQueue.shift(),this._currentChunkOffset=0;else{let s=this._silenceFramesCount>this._silenceThresholdBlocks;if(this._noMoreDataReceived||s){if(this._hasSentEnded||(this.port.postMessage({type:"playback-ended"}),this._hasSentEnded=!0),this._metricsEnabled)try{this.port.postMessage({type:"metrics",data:{state:i.FSM.IDLE,queuedSamples:0,queuedMs:0,maxQueuedMs:Math.round(this._maxQueueSamples/this._sampleRate*1e3),underrunBlocks:this._underrunBlocks,framesProcessed:this._framesProcessed}})}catch{}this.reset();break}else{this._silenceFramesCount++,this._metricsEnabled&&this._underrunBlocks++;break}}if(this._currentChunk){let s=Math.min(u-n,this._currentChunk.length-this._currentChunkOffset),a=this._currentChunk,o=this._currentChunkOffset,_=n,m=this._scale;for(let c=0;c<s;c++)t[_+c]=a[o+c]*m;this._currentChunkOffset+=s,n+=s}}if(n<u&&t.fill(0,n),this._metricsEnabled){this._framesProcessed+=u;let s=0;this._currentChunk&&(s+=Math.max(0,this._currentChunk.length-this._currentChunkOffset));for(let a=0;a<this._bufferQueue.length;a++)s+=this._bufferQueue[a].length;if(s>this._maxQueueSamples&&(this._maxQueueSamples=s),this._framesProcessed-this._lastMetricsSentAtFrame>=this._metricsIntervalFrames){this._lastMetricsSentAtFrame=this._framesProcessed;try{this.port.postMessage({type:"metrics",data:{state:this._state,queuedSamples:s,queuedMs:Math.round(s/this._sampleRate*1e3),maxQueuedMs:Math.round(this._maxQueueSamples/this._sampleRate*1e3),underrunBlocks:this._underrunBlocks,framesProcessed:this._framesProcessed}})}catch{}}}return!0}};registerProcessor("playback-worklet",l);
